"""Classical planners, peers of the learned agents: line of sight and the protection domain (`avoidance`,
`guidance`), the mapping local planner and the oracle (`map_planner`), the Bug planner (`bug`), 3-D line of sight
(`los3d`), and the one deployment chain that wraps a planner's action (`deploy`)."""

"""The goal-conditioned observation convention (Gymnasium-Robotics' GoalEnv) shared by tasks and agents."""

GOAL_KEYS = ("observation", "achieved_goal", "desired_goal")
"""Keys of a goal task's dict observation: what the vehicle senses, where it is, where it should be."""

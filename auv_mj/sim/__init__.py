"""Simulation: the vehicle read from its MJCF, Fossen hydrodynamics inside MuJoCo's step (Python loop and C
kernel), disturbances, the nine-beam sonar, ocean conditions, and the `AUVPhysics` that holds them together."""

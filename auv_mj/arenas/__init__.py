"""Arenas: the MJCF arena convention and its loader, tunnel authoring, procedural arenas and the arena checker
(each built on `auv_mj.sim`)."""

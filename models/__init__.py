"""MJCF files of auv-mj: the vehicle (`auv.xml`) and the arenas (`arenas/`).

This folder is installed as the package `auv_mj.models` so that the XML is found from a wheel too;
use `auv_mj.assets.model_path(name)` rather than building paths by hand.
"""

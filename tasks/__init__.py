"""The dm_control suite of auv-mj (`auv_mj.tasks.suite`) and its Gymnasium face (`auv_mj.tasks.gym_adapter`).

`import auv_mj` registers the Gymnasium ids `auv_mj/*-v0`.
"""

"""How fast auv-mj runs (`auv-mj bench`): measurements of the batched environment beside the physics limit.

Speed, not skill: how well a policy does is `auv_mj.benchmark`.
"""

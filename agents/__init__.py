"""Learned planning and control of Lyu et al. 2023: DDPG, HER-DDPG and the executor (Sec. 3, Table 4)."""

from auv_mj.agents.ddpg import DDPG, DDPGConfig
from auv_mj.agents.her import HerReplayBuffer
from auv_mj.agents.policy import Policy
from auv_mj.agents.replay import Batch, ReplayBuffer

__all__ = ["DDPG", "Batch", "DDPGConfig", "HerReplayBuffer", "Policy", "ReplayBuffer"]

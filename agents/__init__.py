"""Learned planning and control of Lyu et al. 2023: DDPG, HER-DDPG and the executor (Sec. 3, Table 4)."""

from agents.ddpg import DDPG, DDPGConfig
from agents.her import HerReplayBuffer
from agents.policy import Policy
from agents.replay import Batch, ReplayBuffer

__all__ = ["DDPG", "Batch", "DDPGConfig", "HerReplayBuffer", "Policy", "ReplayBuffer"]

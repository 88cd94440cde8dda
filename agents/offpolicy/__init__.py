"""The off-policy stack of Lyu et al. 2023 (Sec. 3, Table 4): DDPG, HER-DDPG, the executor and TD3 on Gymnasium tasks.

Its modules, bottom to top:
- `networks`: the actor and critic MLPs and their one-vector Adam (the normaliser is `auv_mj.agents.normalizer`);
- `replay` and `her`: the replay pool, and hindsight relabelling as a replay-buffer concern;
- `ddpg` and `td3`: the learners, their config dataclasses and their update steps as importable functions;
- `learners`: the learners by name (`auv-mj train AGENT`) and an agent's whole state in a checkpoint
  (`auv_mj.agents.checkpoint`, kinds "ddpg", "her-ddpg", "executor", "td3");
- `collector`: environments stepped, and the actor learnt, in collector processes;
- `train`: the training loop as a library (`train`);
- `policy`: the deterministic policy a trained checkpoint deploys (`Policy.load`).
"""

from auv_mj.agents.offpolicy.ddpg import DDPG, DDPGConfig
from auv_mj.agents.offpolicy.her import HerReplayBuffer
from auv_mj.agents.offpolicy.learners import AGENTS, agent_classes, load_agent, save_agent
from auv_mj.agents.offpolicy.policy import Policy
from auv_mj.agents.offpolicy.replay import Batch, ReplayBuffer
from auv_mj.agents.offpolicy.td3 import TD3, TD3Config
from auv_mj.agents.offpolicy.train import TrainResult, train

__all__ = ["AGENTS", "DDPG", "TD3", "Batch", "DDPGConfig", "HerReplayBuffer", "Policy", "ReplayBuffer", "TD3Config",
           "TrainResult", "agent_classes", "load_agent", "save_agent", "train"]

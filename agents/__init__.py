"""Learned planning and control: two learning stacks over one checkpoint format.

- `auv_mj.agents.offpolicy`: DDPG, HER-DDPG and the executor of Lyu et al. 2023 (Sec. 3, Table 4), and TD3;
- `auv_mj.agents.ppo`: PPO with an optional GRU or LSTM memory, and the planner trained with it;
- `auv_mj.agents.checkpoint`: the one checkpoint format (atomic, weights-only, tagged with its kind) and its one
  loader, `read_checkpoint`;
- `auv_mj.agents.normalizer`: the running input normaliser both stacks use; `auv_mj.agents.baselines`: policies
  that act on observations alone.

The shipped checkpoints are in `checkpoints/` beside this file.
"""

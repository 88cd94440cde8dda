"""PPO with an optional GRU or LSTM memory, on Gymnasium vector envs, and the planner trained with it.

- `ppo`: the algorithm in one file, top to bottom as CleanRL's: config and schedules, actor-critic (an optional
  critic of its own with privileged inputs), rollout, GAE, clipped losses, update (an optional KL limit),
  checkpoint (kind "ppo" of `auv_mj.agents.checkpoint`) and training loop with per-cell logs;
- `gru`: the update's GRU over whole sequences, its backward pass written out (`gru_sequence`);
- `spaces`: one env's spaces as the networks see them (`env_spec`, `flatten_obs`, `env_action`);
- `policy`: the deployable deterministic policy (`PPOPolicy.load`);
- `planner`: the planner learned on the batched training mixture (hard cells oversampled by `cell_weights`), chosen
  on a windowed mean of validations (`train_planner`, `windowed_choice`; `LEARNED_CONFIG`, `LEARNED_MIXTURE`);
- `export`: a training checkpoint's network alone, for `agents/checkpoints/` (`python -m auv_mj.agents.ppo.export`).
"""

from auv_mj.agents.ppo.gru import gru_sequence
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.agents.ppo.ppo import (
    CELLS_LOG_NAME,
    CHECKPOINT_NAME,
    LOG_NAME,
    ActorCritic,
    Collector,
    Episode,
    Minibatch,
    PPOConfig,
    PPOResult,
    Rollout,
    build_model,
    clipped_surrogate,
    gae,
    load_model,
    make_optimizer,
    minibatches,
    ppo_loss,
    read_ppo,
    reset_seeds,
    save_ppo,
    schedule_at,
    scheduled,
    train,
    update,
    value_loss,
)
from auv_mj.agents.ppo.spaces import OBS_KEYS, autoreset_mode, env_action, env_spec, flatten_obs

__all__ = ["CELLS_LOG_NAME", "CHECKPOINT_NAME", "LOG_NAME", "OBS_KEYS", "ActorCritic", "Collector", "Episode",
           "Minibatch", "PPOConfig", "PPOPolicy", "PPOResult", "Rollout", "autoreset_mode", "build_model",
           "clipped_surrogate", "env_action", "env_spec", "flatten_obs", "gae", "gru_sequence", "load_model",
           "make_optimizer", "minibatches", "ppo_loss", "read_ppo", "reset_seeds", "save_ppo", "schedule_at",
           "scheduled", "train", "update", "value_loss"]

"""PPO with an optional GRU or LSTM memory, on Gymnasium vector envs, and the planner trained with it.

- `ppo`: the algorithm, top to bottom as CleanRL's: GAE, the clipped losses, minibatches, the update (an optional KL
  limit) and the training loop;
- `config`: its hyper-parameters (`PPOConfig`) and their schedules;
- `model`: the actor-critic (an optional GRU/LSTM memory, an optional critic of its own with privileged inputs);
- `gru`: the update's GRU over whole sequences, its backward pass written out (`gru_sequence`);
- `rollout`: the `Collector` that steps the env into a `Rollout`, through episode ends and autoresets;
- `logs`: progress.csv, cells.csv (per cell of the env) and TensorBoard;
- `checkpoint`: the run's checkpoint, kind "ppo" of `auv_mj.agents.checkpoint` (`save_ppo`, `read_ppo`, `load_model`);
- `spaces`: one env's spaces as the networks see them (`env_spec`, `flatten_obs`, `env_action`);
- `policy`: the deployable deterministic policy (`PPOPolicy.load`);
- `planner`: the planner learned on the batched training mixture (hard cells oversampled by `cell_weights`), chosen
  on a windowed mean of validations (`train_planner`, `windowed_choice`; `LEARNED_CONFIG`, `LEARNED_MIXTURE`);
- `export`: a training checkpoint's network alone, for `agents/checkpoints/` (`python -m auv_mj.agents.ppo.export`).
"""

from auv_mj.agents.ppo.checkpoint import CHECKPOINT_NAME, load_model, read_ppo, save_ppo
from auv_mj.agents.ppo.config import PPOConfig, schedule_at, scheduled
from auv_mj.agents.ppo.gru import gru_sequence
from auv_mj.agents.ppo.logs import CELLS_LOG_NAME, LOG_NAME
from auv_mj.agents.ppo.model import ActorCritic, build_model
from auv_mj.agents.ppo.policy import PPOPolicy
from auv_mj.agents.ppo.ppo import (
    Minibatch,
    PPOResult,
    advantages_of,
    clipped_surrogate,
    gae,
    make_optimizer,
    minibatches,
    ppo_loss,
    reset_seeds,
    train,
    update,
    value_loss,
)
from auv_mj.agents.ppo.rollout import Collector, Episode, Rollout
from auv_mj.agents.ppo.spaces import OBS_KEYS, autoreset_mode, env_action, env_spec, flatten_obs

__all__ = ["CELLS_LOG_NAME", "CHECKPOINT_NAME", "LOG_NAME", "OBS_KEYS", "ActorCritic", "Collector", "Episode",
           "Minibatch", "PPOConfig", "PPOPolicy", "PPOResult", "Rollout", "advantages_of", "autoreset_mode",
           "build_model", "clipped_surrogate", "env_action", "env_spec", "flatten_obs", "gae", "gru_sequence",
           "load_model", "make_optimizer", "minibatches", "ppo_loss", "read_ppo", "reset_seeds", "save_ppo",
           "schedule_at", "scheduled", "train", "update", "value_loss"]

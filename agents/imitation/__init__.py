"""Imitation of a privileged teacher (issue 51): DAgger for a recurrent student (`auv_mj.agents.imitation.dagger`)."""

from auv_mj.agents.imitation.dagger import (
    CELLS_LOG_NAME,
    CHECKPOINT_NAME,
    LOG_NAME,
    STUDENT_NAME,
    DaggerConfig,
    DaggerResult,
    Sequences,
    collect,
    episodes_validator,
    evaluate_student,
    finetune,
    fit,
    imitation_loss,
    student_spec,
    train_dagger,
)

__all__ = ["CELLS_LOG_NAME", "CHECKPOINT_NAME", "LOG_NAME", "STUDENT_NAME", "DaggerConfig", "DaggerResult",
           "Sequences", "collect", "episodes_validator", "evaluate_student", "finetune", "fit", "imitation_loss",
           "student_spec", "train_dagger"]

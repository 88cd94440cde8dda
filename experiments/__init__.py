"""Experiments of auv-mj, kept beside the package rather than in it (none of them is installed): the paper
reproduction's sections (`experiments.report`, run by `auv-mj reproduce` from a checkout), the training-speed peer
(`experiments.sb3_peer`), and the programs that made shipped gains, figures and selections (experiments/README.md)."""

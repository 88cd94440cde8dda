"""How saturated a DAgger run's labels are: the share of its teacher's actions at the edge of the action box.

    python docs/runs/planner-learned/label_saturation.py runs/planning-mix/dagger-map-mapteacher-seed0/dagger.pt

Reads the aggregate a DAgger run keeps (`dagger.pt`: data.labels, data.valid, data.teacher_drove) and prints, over
the valid labelled steps, the share of heading labels with |a1| > 0.95, of speed labels a0 > 0.95, and the heading
labels' histogram; apart for the steps the teacher drove (round 0) and the steps the student drove.
"""

from __future__ import annotations

import sys

import numpy as np
import torch

EDGES = [-1.01, -0.95, -0.5, -0.05, 0.05, 0.5, 0.95, 1.01]


def main(path: str) -> None:
    tensors = torch.load(path, weights_only=True, map_location="cpu")["tensors"]
    valid = tensors["data.valid"].numpy() > 0
    labels = tensors["data.labels"].numpy()[valid]
    teacher = tensors["data.teacher_drove"].numpy()[valid] > 0
    print(f"{len(labels)} labelled steps ({teacher.mean():.3f} of them driven by the teacher)")
    for name, rows in (("all", slice(None)), ("teacher drove", teacher), ("student drove", ~teacher)):
        heading, speed = labels[rows, 1], labels[rows, 0]
        print(f"{name}: heading |a1| > 0.95 {np.mean(np.abs(heading) > 0.95):.3f}, |a1| < 0.05 "
              f"{np.mean(np.abs(heading) < 0.05):.3f}; speed a0 > 0.95 {np.mean(speed > 0.95):.3f}")
    shares = np.histogram(labels[:, 1], bins=EDGES)[0] / len(labels)
    print("heading labels by bin", ", ".join(f"[{a:+.2f}, {b:+.2f}): {s:.3f}" for a, b, s in
                                            zip(EDGES[:-1], EDGES[1:], shares, strict=True)))


if __name__ == "__main__":
    main(sys.argv[1])

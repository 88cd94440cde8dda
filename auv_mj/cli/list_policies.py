"""`auv-mj policies`: the policy registry (`auv_mj.zoo.registry.POLICIES`) as a table."""

from __future__ import annotations

import argparse

from auv_mj.zoo import registry as policies


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """--markdown prints the table of docs/policies.md."""
    parser.add_argument("--markdown", action="store_true", help="print the table as Markdown (docs/policies.md's)")


def run(args: argparse.Namespace) -> int:
    """Prints every registered policy with its family, the tasks it runs on (domains and kind), executor,
    protection domain and description."""
    if args.markdown:
        print(policies.markdown_table())
        return 0
    width = max(map(len, policies.POLICIES))
    for role, title in policies.ROLES.items():
        print(f"{title}:")
        for name, spec in policies.POLICIES.items():
            if spec.role == role:
                print(f"  {name:{width}s}  [{spec.family}, {policies.runs_on_label(spec)}] {spec.description}")
        print()
    print(f"Also: a checkpoint path, or NAME=PATH for "
          f"{', '.join(n for n, s in policies.POLICIES.items() if s.accepts_path)}.")
    return 0

"""Finished episodes kept as they end, so that an interrupted `evaluate` or `benchmark` resumes where it stopped.

A journal is an append-only JSON Lines file. Its first line names the run: the data that decides which episodes it
runs and what they give (the policy, the tasks or cells, episodes, seeds, options, the suite's version). Every
further line is one finished episode, its key and its metrics, written whole with one `write` and forced to disk
(`fsync`) before the run goes on. A kill can cut only the line being written, the last one, which has no newline
yet: reading drops it and the next run writes over it. So every line a journal holds is an episode that ended, and
Python's `json` writes floats in their shortest exact form: an episode read back is the one that was run, bit for
bit, and a resumed run gives the uninterrupted run's results.

A journal of another run (any field of its first line differs) is refused (`JournalMismatch`, naming the file and
the fields) unless `force`, which starts it afresh. One run at a time: the file is locked while it is open.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
from pathlib import Path
from typing import Any

JOURNAL = "journal.jsonl"
"""The journal's file name in an output folder (`auv-mj benchmark --out DIR`)."""
FORMAT = 1
"""The journal's format version, part of its first line."""


class JournalMismatch(ValueError):
    """A journal that holds another run's episodes (or is no journal)."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a run: how many episodes were kept in the run's journal (None: the run kept none) and how
    many the run has. A KeyboardInterrupt still, so that code that stops on Ctrl-C stops on it."""

    def __init__(self, journal: Path | None, kept: int, total: int):
        super().__init__(f"interrupted: {kept} of {total} episodes kept in {journal}" if journal is not None
                         else f"interrupted after {kept} of {total} episodes; no journal kept them")
        self.journal, self.kept, self.total = journal, kept, total


def policy_identity(policy_name: str) -> dict:
    """What names a policy in a journal's first line: its name, and the SHA-256 of its file when it names one (a
    checkpoint or an SB3 zip), so that a retrained checkpoint at the same path is another run."""
    path = Path(policy_name)
    identity: dict[str, Any] = {"policy": policy_name}
    if path.is_file():
        identity["policy_sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
    return identity


def _plain(data: Any) -> Any:
    """`data` as JSON gives it back (tuples become lists), so that a run's identity compares with a stored one."""
    return json.loads(json.dumps(data, sort_keys=True))


class Journal:
    """An open journal: `episodes` ({key: metrics}) holds those a previous run kept; `add` keeps one more.

    Keys are tuples of JSON scalars (task and episode index, cell and seed); metrics are JSON-able dicts.
    """

    def __init__(self, path: str | Path, run: dict, *, force: bool = False):
        self.path = Path(path)
        self.run = _plain(run)
        self.episodes: dict[tuple, dict] = {}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(self.path, "a+b")  # noqa: SIM115 (held open for the run, closed by `close`)
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.close()
            raise JournalMismatch(f"{self.path} is in use by another run (it holds that run's episodes)") from None
        try:
            self._read(force)
        except BaseException:
            self.close()
            raise

    def _read(self, force: bool) -> None:
        self._file.seek(0)
        content = self._file.read()
        lines = content.split(b"\n")
        whole = lines[:-1]  # the last piece is empty, or a line cut short by a kill
        if not whole and (not content or content.startswith(b'{"journal"')):  # new, or its first line was cut
            self._restart()
            return
        header = _parse(whole[0]) if whole else None
        if header != {"journal": FORMAT, "run": self.run}:
            if not force:
                raise JournalMismatch(self._mismatch(header))
            self._restart()
            return
        for number, line in enumerate(whole[1:], start=2):
            entry = _parse(line)
            if entry is None or set(entry) != {"key", "metrics"}:
                raise JournalMismatch(f"{self.path}: line {number} is not an episode of this journal; move the "
                                      "file away, or pass force=True (`--force`) to start afresh there")
            self.episodes[tuple(entry["key"])] = entry["metrics"]
        kept = sum(len(line) + 1 for line in whole)
        if kept < len(content):  # drop the cut line, so that the next episode starts a line of its own
            self._file.truncate(kept)
            self._sync()

    def _mismatch(self, header: dict | None) -> str:
        stored = header.get("run") if header is not None else None
        if not isinstance(stored, dict) or header is None or header.get("journal") != FORMAT:
            return (f"{self.path} is no episode journal of this auv-mj (format {FORMAT}); move it away, or pass "
                    "force=True (`--force`) to start afresh there")
        fields = sorted(k for k in set(stored) | set(self.run) if stored.get(k) != self.run.get(k))
        differences = "; ".join(f"{k}: {json.dumps(stored.get(k))} there, {json.dumps(self.run.get(k))} here"
                                for k in fields)
        return (f"{self.path} holds the episodes of another run ({differences}); run that command to resume it, "
                "choose another output, or pass force=True (`--force`) to start afresh there")

    def _restart(self) -> None:
        self._file.truncate(0)
        self._append({"journal": FORMAT, "run": self.run})  # `_plain`: keys sorted

    def _append(self, data: dict) -> None:
        self._file.seek(0, os.SEEK_END)
        self._file.write(json.dumps(data).encode() + b"\n")  # keys in their order: the results keep it
        self._sync()

    def _sync(self) -> None:
        self._file.flush()
        os.fsync(self._file.fileno())

    def add(self, key: tuple, metrics: dict) -> None:
        """Keeps one finished episode: on disk before this returns."""
        self._append({"key": list(key), "metrics": metrics})
        self.episodes[tuple(key)] = metrics

    def kept(self) -> int:
        """How many episodes the file holds now, counted on disk (what a resumed run will find): Ctrl-C can fall
        between an episode's line reaching the file and `episodes` taking it, so that is not counted there."""
        self._sync()
        self._file.seek(0)
        return max(self._file.read().count(b"\n") - 1, 0)  # whole lines, less the run's first line

    def close(self) -> None:
        """Releases the file (and its lock); the episodes stay in it."""
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _parse(line: bytes) -> dict | None:
    """One complete line of a journal, or None where it is not a JSON object."""
    try:
        data = json.loads(line)
    except ValueError:
        return None
    return data if isinstance(data, dict) else None

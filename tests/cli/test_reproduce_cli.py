"""``chronofuse reproduce ...``: the source paper reaches the experiment, and nothing is written into docs/ unasked."""

from __future__ import annotations

import typer

from chronofuse.cli.common import run_reproduction
from chronofuse.cli.main import build_app


def _fake(out, *, quick, progress, **kwargs):
    return {"quick": quick, **kwargs}


def test_the_seed_reaches_the_experiment_only_when_given(tmp_path):
    assert run_reproduction("x", _fake, tmp_path, quick=True, json_out=False) == {"quick": True}
    assert run_reproduction("x", _fake, tmp_path, quick=False, json_out=False, seed=7) == {"quick": False, "seed": 7}


def test_no_command_writes_into_docs_by_default():
    command = typer.main.get_command(build_app())

    def leaves(group, path=()):
        for name, sub in getattr(group, "commands", {}).items():
            yield from leaves(sub, (*path, name)) if hasattr(sub, "commands") else [((*path, name), sub)]

    defaults = {" ".join(path): str(p.default) for path, cmd in leaves(command) for p in cmd.params
                if p.name == "out" and p.default is not None}
    assert defaults and not [c for c, d in defaults.items() if d.startswith("docs")], defaults

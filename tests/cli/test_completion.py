"""Shell completion: ``chronofuse --show-completion bash`` prints a script that, sourced into a real bash,
completes subcommands and options through the program itself (Typer's ``_CHRONOFUSE_COMPLETE`` protocol).

bash runs the script's completion function the way readline does (``COMP_WORDS``/``COMP_CWORD`` set, the
function called with the command's name); the program it calls is a ``chronofuse`` on ``PATH`` that runs
this tree's ``chronofuse.cli.main:main`` in this interpreter, as the console script does.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"


@pytest.fixture(scope="module")
def program(tmp_path_factory) -> dict:
    """A ``chronofuse`` executable on a private PATH, and the environment to run bash in."""
    bin_dir = tmp_path_factory.mktemp("bin")
    exe = bin_dir / "chronofuse"
    exe.write_text(f"#!/bin/sh\nexec {sys.executable} -c 'import sys; from chronofuse.cli.main import main; "
                   f"sys.argv[0] = \"chronofuse\"; main()' \"$@\"\n")
    exe.chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
           "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
           "SHELL": shutil.which("bash") or "/bin/bash"}
    script = subprocess.run([str(exe), "--show-completion", "bash"], capture_output=True, text=True, env=env,
                            timeout=60)
    assert script.returncode == 0, script.stderr
    assert "complete " in script.stdout and "_CHRONOFUSE_COMPLETE" in script.stdout
    path = bin_dir / "chronofuse-completion.bash"
    path.write_text(script.stdout)
    return {"env": env, "script": path}


def _complete(program: dict, words: list[str]) -> list[str]:
    """What bash's completion offers for the command line ``words`` (the last one being typed)."""
    quoted = " ".join(f"'{w}'" for w in words)
    line = (f"source '{program['script']}'; COMP_WORDS=({quoted}); COMP_CWORD={len(words) - 1}; "
            "_chronofuse_completion chronofuse; printf '%s\\n' \"${COMPREPLY[@]}\"")
    done = subprocess.run(["bash", "--norc", "--noprofile", "-c", line], capture_output=True, text=True,
                          env=program["env"], timeout=60)
    assert done.returncode == 0, done.stderr
    return [w for w in done.stdout.splitlines() if w]


def test_the_bash_script_completes_a_subcommand(program):
    assert _complete(program, ["chronofuse", "det"]) == ["detect"]
    # a prefix two subcommands share offers both, and nothing else
    assert sorted(_complete(program, ["chronofuse", "s"])) == ["simulate", "stability", "swarm"]


def test_the_bash_script_completes_a_subcommands_option(program):
    assert _complete(program, ["chronofuse", "stability", "--ma"]) == ["--mask"]
    assert "--out" in _complete(program, ["chronofuse", "run", "--"])


def test_a_word_no_command_starts_with_completes_to_nothing(program):
    assert _complete(program, ["chronofuse", "xyz"]) == []

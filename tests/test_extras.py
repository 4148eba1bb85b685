"""A command that needs an optional part which is not installed says so in one line naming the extra, and
exits 2: run in a fresh interpreter where the part cannot be imported."""

import subprocess
import sys
import textwrap

import pytest

from chronofuse.extras import EXTRAS, MissingExtraError, require

BLOCK = textwrap.dedent("""
    import sys
    class Block:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in {blocked!r}:
                raise ImportError(f"No module named {{name!r}} (blocked)")
    sys.meta_path.insert(0, Block())
    from chronofuse.cli.main import main
    sys.argv = ["chronofuse"] + {argv!r}
    main()
""")


def _run_without(blocked: set, argv: list, tmp_path) -> subprocess.CompletedProcess:
    code = BLOCK.format(blocked=sorted(blocked), argv=argv)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300)


@pytest.mark.parametrize("blocked, argv, extra", [
    ({"torch"}, ["swarm", "train", "--quick", "--out", "nets"], "ml"),
    ({"dask", "distributed"}, ["swarm", "sweep", "--param", "velocity", "--values", "100,200"], "dask"),
    ({"serial"}, ["monitor", "serial:/dev/ttyUSB9@9600", "--duration", "5"], "live"),
])
def test_a_command_without_its_extra_exits_2_with_one_line_naming_it(blocked, argv, extra, tmp_path):
    result = _run_without(blocked, argv, tmp_path)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and f"pip install 'chronofuse[{extra}]'" in lines[0], result.stderr
    assert "Traceback" not in result.stderr and not (tmp_path / "nets").exists()


def test_require_returns_the_module_when_it_is_there_and_names_the_extra_when_not():
    assert require("serial", "x").__name__ == "serial"
    assert set(EXTRAS) >= {"torch", "distributed", "serial"}
    EXTRAS["_chronofuse_absent"] = ("absent-dist", "absent")
    try:
        with pytest.raises(MissingExtraError, match=r"^y needs absent-dist, which is not installed: pip install "
                                                    r"'chronofuse\[absent\]'$"):
            require("_chronofuse_absent", "y")
    finally:
        del EXTRAS["_chronofuse_absent"]

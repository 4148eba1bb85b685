"""Every option of every subcommand, collected from the command tree: one name means one thing with one unit.

The table of options is :data:`chronofuse.cli.flags.FLAGS` (meaning, kind, unit, the config fields it sets).
Each option the program offers must be in it, be of its kind (a switch, a count, a number, a text, a path)
in every subcommand, and carry its unit in its help as ``(unit)`` or in its name; the options every command
shares (``--json``, ``--quiet``, ``--seed``, ``--out``) are where they make sense.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from chronofuse.cli.flags import FLAGS

from _helpers import command_tree, option_type  # noqa: E402

#: Python types of an option's value for each kind of the table.
KIND_TYPES = {"switch": {bool}, "count": {int}, "number": {int, float}, "text": {str}, "path": {Path}}
#: Commands that draw no random numbers (so no --seed) and write no report (so no --out).
NO_SEED = {"stability", "detect", "inspect", "monitor", "log"}
NO_OUT = {"stability", "detect"}  # stability writes its plot with --plot; detect prints its document


COMMANDS = command_tree()
OPTIONS = [(command, p) for command, cmd in COMMANDS.items() for p in cmd.params if p.param_type_name == "option"]
_type = option_type


def _name(param) -> str:
    (name,) = param.opts  # one name per option: no aliases for the same idea
    return name


def test_the_tree_holds_every_subcommand():
    assert len(COMMANDS) >= 18 and {"detect", "monitor", "swarm sweep", "reproduce gnssdo"} <= set(COMMANDS)


@pytest.mark.parametrize("command, param", OPTIONS, ids=[f"{c} {'/'.join(p.opts)}" for c, p in OPTIONS])
def test_an_option_is_in_the_table_of_its_kind_with_its_unit(command, param):
    name = _name(param)
    assert name in FLAGS, f"{command} {name}: not in chronofuse.cli.flags.FLAGS (a new name, or another for an idea that has one)"
    flag = FLAGS[name]
    assert _type(param) in KIND_TYPES[flag.kind], f"{command} {name}: {_type(param)} is not a {flag.kind}"
    if flag.unit is not None:
        in_name = name.lower().endswith("-" + flag.unit.lower())
        in_help = re.search(r"\(" + re.escape(flag.unit) + r"[,;)]", param.help or "")
        assert in_name or in_help, f"{command} {name}: its help does not say its unit as ({flag.unit}): {param.help!r}"


def test_one_name_has_one_kind_and_one_unit_across_the_subcommands():
    seen: dict[str, set] = {}
    for command, param in OPTIONS:
        flag = FLAGS[_name(param)]
        seen.setdefault(_name(param), set()).add((flag.kind, flag.unit, _type(param) is bool))
    assert {name: kinds for name, kinds in seen.items() if len(kinds) > 1} == {}


def test_the_table_names_each_idea_once_and_every_entry_is_offered_somewhere():
    meanings = [flag.meaning for flag in FLAGS.values()]
    assert len(set(meanings)) == len(meanings)
    offered = {_name(p) for _, p in OPTIONS}
    assert sorted(set(FLAGS) - offered) == []


def test_json_quiet_seed_and_out_are_wherever_they_make_sense():
    names = {command: {_name(p) for p in cmd.params if p.param_type_name == "option"} for command, cmd in COMMANDS.items()}
    assert [c for c, n in names.items() if not {"--json", "--quiet"} <= n] == []
    assert [c for c, n in names.items() if c.split()[0] not in NO_SEED and "--seed" not in n] == []
    assert [c for c, n in names.items() if c not in NO_OUT and "--out" not in n] == []


def test_the_names_that_meant_two_things_or_one_thing_twice_are_gone():
    # detect --train seconds vs monitor --training epochs; --speed m/s vs a replay factor; --algorithm vs
    # --algorithms; --station vs --receiver; --export vs --out; --preset vs --oscillator; --scenario for
    # three kinds of environment
    offered = {_name(p) for _, p in OPTIONS}
    assert offered.isdisjoint({"--training", "--algorithms", "--receiver", "--export", "--preset", "--scenario"})
    speeds = {c: p.help for c, p in OPTIONS if _name(p) == "--speed"}
    assert set(speeds) == {"position"} and "(m/s" in speeds["position"]

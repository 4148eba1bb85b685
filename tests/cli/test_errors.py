"""Bad input is exit 2 in one line naming the option; anything else is a bug and says so (exit 70).

The library names config fields (``{rate_hz} == 0, must be > 0``, :class:`~chronofuse.validation.InputError`);
the command line writes each as the option that sets it, from the one table in :mod:`chronofuse.cli.flags`.
"""

from __future__ import annotations

import pytest
from pydantic import BaseModel, Field, ValidationError
from typer.testing import CliRunner

import chronofuse.models.oscillator as oscillator_models
from chronofuse.cli.common import describe
from chronofuse.cli.flags import FLAG_OF_FIELD, FLAGS, label
from chronofuse.cli.main import EXIT_BUG, app
from chronofuse.validation import InputError, check_scalar

runner = CliRunner()


def test_an_input_error_names_its_field_in_the_library_and_its_option_on_the_command_line():
    with pytest.raises(InputError) as caught:
        check_scalar(0.0, "rate_hz", min_val=0.0, include_min=False)
    assert str(caught.value) == "rate_hz == 0.0, must be > 0.0"
    assert describe(caught.value) == "--rate == 0.0, must be > 0.0"
    assert isinstance(caught.value, ValueError)  # code catching ValueError keeps working


def test_a_field_whose_option_has_another_unit_is_named_with_both():
    assert label("max_time_acc_s") == "max_time_acc_s (--max-tacc-ns)"
    assert label("duration_s") == "--duration"
    assert label("not_a_field_of_any_option") == "not_a_field_of_any_option"


def test_every_config_field_is_set_by_one_option_only():
    owners: dict[str, list[str]] = {}
    for name, flag in FLAGS.items():
        for field in flag.fields:
            owners.setdefault(field, []).append(name)
    assert {f: o for f, o in owners.items() if len(o) > 1} == {}
    assert len(FLAG_OF_FIELD) == sum(len(flag.fields) for flag in FLAGS.values())


def test_a_value_the_library_refuses_is_exit_2_in_one_line_naming_the_options(tmp_path):
    result = runner.invoke(app, ["simulate", "oscillator", "--duration", "1", "--out", str(tmp_path / "o.csv")])
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == ["error: --duration * --rate == 1.0, must round to at least 2 steps"]


def test_a_path_the_system_refuses_is_exit_2_naming_the_path(tmp_path):
    missing = tmp_path / "nowhere.csv"
    result = runner.invoke(app, ["stability", str(missing), "--rate", "1"])
    assert result.exit_code == 2, result.output
    assert len(result.stderr.splitlines()) == 1 and str(missing) in result.stderr


def test_a_config_validation_error_names_the_option_of_its_field():
    class Config(BaseModel):
        rate_hz: float = Field(gt=0)

    with pytest.raises(ValidationError) as caught:
        Config(rate_hz=-1.0)
    assert describe(caught.value) == "--rate == -1.0, must be > 0"  # worded as the library words its own


def _broken(*args, **kwargs):
    raise ValueError("an internal invariant broke")


def test_a_value_error_that_is_not_an_input_error_is_reported_as_a_bug_not_as_bad_input(monkeypatch, tmp_path):
    monkeypatch.setattr(oscillator_models, "simulate_oscillator", _broken)  # the command imports it when run
    result = runner.invoke(app, ["simulate", "oscillator", "--out", str(tmp_path / "o.csv")])
    assert result.exit_code == EXIT_BUG != 2
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and "a bug in chronofuse, not in your input" in lines[0]
    assert "ValueError: an internal invariant broke" in lines[0] and "--debug" in lines[0]


def test_debug_prints_the_traceback_of_a_bug(monkeypatch, tmp_path):
    monkeypatch.setattr(oscillator_models, "simulate_oscillator", _broken)  # the command imports it when run
    result = runner.invoke(app, ["--debug", "simulate", "oscillator", "--out", str(tmp_path / "o.csv")])
    assert result.exit_code == EXIT_BUG
    assert "Traceback (most recent call last)" in result.stderr and "_broken" in result.stderr


def test_a_field_is_written_as_an_option_only_of_the_command_that_has_that_option():
    import typer

    from chronofuse.cli.main import build_app

    program = typer.main.get_command(build_app())
    error = InputError("{interval_s} == 0.3, must divide 1 s", fields=("interval_s",))
    with program.commands["swarm"].commands["run"].make_context("run", []):
        assert describe(error) == "--interval == 0.3, must divide 1 s"
    with program.commands["detect"].make_context("detect", ["x.csv"]):  # detect has no --interval
        assert describe(error) == "interval_s == 0.3, must divide 1 s"

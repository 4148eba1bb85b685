"""Residual networks: numpy inference equals torch, training is reproducible, model files are checked."""

import dataclasses

import numpy as np
import pytest
from typer.testing import CliRunner

torch = pytest.importorskip("torch")

from chronofuse.cli.main import app  # noqa: E402
from chronofuse.sync.residual import ResidualConfig, ResidualNetwork, load_residual_network, parameter_count  # noqa: E402
from chronofuse.validation import ChronofuseError  # noqa: E402


def _data(n, window, seed):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, window, 9))
    y = 0.8 * np.tanh(X[:, -1, 2]) + 0.3 * X[:, -1, 4] + 0.05 * rng.standard_normal(n)
    return X, y


@pytest.fixture(scope="module")
def bp():
    X, y = _data(3000, 1, 0)
    Xv, yv = _data(600, 1, 1)
    return ResidualNetwork(ResidualConfig(epochs=15, batch=128, seed=3)).fit(X, y, Xv, yv)


def test_parameter_counts_are_the_architectures():
    assert parameter_count(ResidualConfig()) == 9 * 32 + 32 + 32 + 1
    lstm = ResidualConfig(kind="lstm", window=16)
    assert parameter_count(lstm) == 4 * 32 * (9 + 32) + 8 * 32 + 33


def test_numpy_inference_of_the_bp_network_equals_torch(bp):
    X, _ = _data(200, 1, 5)
    with torch.no_grad():
        ref = bp.model_(torch.as_tensor(X[:, 0, :], dtype=torch.float32)).numpy()[:, 0]
    np.testing.assert_allclose(bp.predict_ns(X), ref, rtol=1e-5, atol=1e-6)


def test_the_network_learns_the_target_better_than_its_mean(bp):
    X, y = _data(1000, 1, 7)
    assert np.sqrt(np.mean((bp.predict_ns(X) - y) ** 2)) < 0.5 * y.std()


def test_training_is_reproducible_from_its_seed(bp):
    X, y = _data(3000, 1, 0)
    Xv, yv = _data(600, 1, 1)
    again = ResidualNetwork(ResidualConfig(epochs=15, batch=128, seed=3)).fit(X, y, Xv, yv)
    for (name, a), (_, b) in zip(bp.model_.state_dict().items(), again.model_.state_dict().items()):
        assert torch.equal(a, b), name


def test_a_saved_model_loads_back_and_a_mismatching_file_is_refused(bp, tmp_path):
    path = bp.save(tmp_path / "bp.pt")
    loaded = load_residual_network(path, chain=bp.config.chain)
    X, _ = _data(50, 1, 9)
    np.testing.assert_array_equal(loaded.predict_ns(X), bp.predict_ns(X))
    doc = torch.load(path, weights_only=True)
    doc["config"]["hidden"] = 16
    torch.save(doc, tmp_path / "bad.pt")
    with pytest.raises(ChronofuseError, match="do not match the configuration"):
        load_residual_network(tmp_path / "bad.pt")
    doc = torch.load(path, weights_only=True)
    doc["state_dict"]["0.bias"] = doc["state_dict"]["0.bias"] + 1.0
    torch.save(doc, tmp_path / "tampered.pt")
    with pytest.raises(ChronofuseError, match="digest"):
        load_residual_network(tmp_path / "tampered.pt")
    with pytest.raises(ChronofuseError, match="trained behind chain"):
        load_residual_network(path, chain={**bp.config.chain, "urt_mode": "paper"})


def test_the_swarm_report_names_a_model_file_by_its_name_digest_and_training_command_not_its_path(bp, tmp_path):
    from chronofuse.experiments.swarm_reproduce import _models_text, model_records
    from chronofuse.experiments.swarm_training import training_record

    where = tmp_path / "machine-only" / "bp.pt"
    bp.save(where, training=training_record(seed=4))
    records = model_records({"bp": where})
    assert records == {"bp": {"file": "bp.pt", "sha256": bp.digest_, "trained_by": "chronofuse swarm train --seed 4"}}
    text = _models_text(records)
    assert str(tmp_path) not in text and "machine-only" not in text
    assert text == f"bp = bp.pt (weights' SHA-256 {bp.digest_[:12]}..., written by `chronofuse swarm train --seed 4`), " \
                   "given as --model FILE"
    # a file saved without its training names none; an old swarm.json's path shows as the file's name
    bp.save(tmp_path / "plain.pt")
    assert model_records({"bp": tmp_path / "plain.pt"})["bp"]["trained_by"] is None
    assert _models_text({"bp": "/tmp/x/y/bp.pt"}) == "bp = bp.pt, given as --model FILE"
    # the digest names the content: other weights, another digest
    doc = torch.load(where, weights_only=True)
    doc["state_dict"]["0.bias"] = doc["state_dict"]["0.bias"] + 1.0
    retrained = ResidualNetwork(bp.config)
    model = load_residual_network(where).model_
    model.load_state_dict(doc["state_dict"])
    retrained._set_model(model)
    assert retrained.digest_ != bp.digest_
    assert training_record(seed=0, quick=True, urt_mode="paper")["command"] == \
        "chronofuse swarm train --quick --seed 0 --urt-mode paper"


def test_the_cli_refuses_a_mismatching_model_file_in_one_line(bp, tmp_path):
    doc = torch.load(bp.save(tmp_path / "bp.pt"), weights_only=True)
    doc["config"]["hidden"] = 8
    torch.save(doc, tmp_path / "bad.pt")
    result = CliRunner().invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc-kf-bp", "--model", str(tmp_path / "bad.pt"),
                                      "--exchanges", "50", "--trials", "1"])
    assert result.exit_code == 2
    lines = [x for x in result.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --model"), result.stderr
    missing = CliRunner().invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc-kf-bp", "--exchanges", "50"])
    assert missing.exit_code == 2 and "--model" in missing.stderr


def test_the_chain_with_a_network_streams_what_its_batch_run_gives(bp):
    from chronofuse.estimation.interface import compare_streaming_to_batch
    from chronofuse.experiments.swarm import LinkScenario, knowledge_of, simulate_scenario
    from chronofuse.sync.base import measurement_array
    from chronofuse.sync.registry import make_algorithm

    sc = LinkScenario(exchanges=120)
    alg = make_algorithm("rtt-rvc-kf-bp", knowledge_of(sc, None), networks={"bp": bp}).fit()
    assert alg.warmup_steps_ == 72
    assert compare_streaming_to_batch(alg, measurement_array(simulate_scenario(sc, 2, 3)[0])) == []
    with pytest.raises(ValueError, match="needs a trained bp network"):
        make_algorithm("rtt-rvc-kf-bp", knowledge_of(sc, None))
    assert dataclasses.asdict(bp.config)["chain"]["urt_mode"] == "calibrated"

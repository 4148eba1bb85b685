"""Residual networks of the paper's chain (the swarm paper's section 2.2.2, eqs. 38-46): BP 9-32-1 and an LSTM.

Both predict the Kalman filter's residual ``eps_true - eps_KF`` (ns) from the nine offset-invariant inputs
of :data:`~chronofuse.sync.chain.FEATURES` (the paper's eq. 38, changed so that no input carries the
absolute offset); the chain adds the prediction clipped to +-5 ns after its warm-up (eq. 46 and
pseudo-code lines 18-28).

* **BP**: ``9 -> 32 (tanh) -> 1`` (eqs. 39-43), loss ``mean((y_hat - y)^2) + lambda (|W1|^2 + |W2|^2)``
  (eq. 44), trained by Adam with early stopping on the validation split. Inference runs in numpy from
  the trained weights (:meth:`ResidualNetwork.predict_residual_s`), checked against torch.
* **LSTM** (the paper's baseline, section 4.6): one LSTM layer of 32 over the last ``window``
  exchanges' inputs, a linear head on its last output, the same loss (lambda on every weight matrix).

Training is reproducible: ``torch.manual_seed(config.seed)`` and a seeded shuffling generator; CPU by
default, the GPU when ``device="auto"`` finds one. A model file holds its configuration, its weights
and a SHA-256 digest of the weights; :func:`load_residual_network` refuses a file whose weights do not
fit its configuration or whose digest differs, and one trained for another chain configuration.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from chronofuse.sync.chain import FEATURES
from chronofuse.validation import ChronofuseError, InputError, check_choice, check_scalar

__all__ = ["ResidualConfig", "ResidualNetwork", "load_residual_network", "parameter_count"]

_FORMAT = 2  # 2: offset-invariant inputs (files of format 1 learnt the offset's size and are refused)


@dataclass(frozen=True)
class ResidualConfig:
    """What a residual network is: ``kind`` ("bp" or "lstm"), ``hidden`` units, ``window`` exchanges
    of inputs (1 for BP), ``l2`` (lambda of eq. 44), ``learning_rate``, ``epochs`` (at most),
    ``patience`` (early stopping), ``batch``, ``seed``, ``device`` ("cpu", "cuda" or "auto"), and
    ``chain``: the chain configuration the network was trained behind (light_time, urt_mode)."""

    kind: str = "bp"
    hidden: int = 32
    window: int = 1
    l2: float = 1e-5
    learning_rate: float = 3e-3
    epochs: int = 40
    patience: int = 6
    batch: int = 1024
    seed: int = 0
    device: str = "cpu"
    chain: dict = field(default_factory=lambda: {"light_time": "paper", "urt_mode": "calibrated"})
    features: tuple = FEATURES

    def __post_init__(self):
        check_choice(self.kind, "kind", ("bp", "lstm"))
        check_scalar(self.hidden, "hidden", min_val=1, integer=True)
        check_scalar(self.window, "window", min_val=1, integer=True)
        if self.kind == "bp" and self.window != 1:
            raise ValueError(f"window == {self.window}, must be 1 for the BP network")
        check_scalar(self.l2, "l2", min_val=0.0)
        check_scalar(self.learning_rate, "learning_rate", min_val=0.0, include_min=False)
        check_scalar(self.epochs, "epochs", min_val=1, integer=True)
        check_scalar(self.batch, "batch", min_val=1, integer=True)
        check_choice(self.device, "device", ("cpu", "cuda", "auto"))
        object.__setattr__(self, "features", tuple(self.features))


def _torch():
    from chronofuse.extras import require

    return require("torch", "the residual networks (BP, LSTM)")


def _build(config: ResidualConfig):
    torch = _torch()
    nn = torch.nn
    n_in = len(config.features)
    if config.kind == "bp":
        return nn.Sequential(nn.Linear(n_in, config.hidden), nn.Tanh(), nn.Linear(config.hidden, 1))

    class _Lstm(nn.Module):
        def __init__(self):
            super().__init__()
            self.lstm = nn.LSTM(n_in, config.hidden, batch_first=True)
            self.head = nn.Linear(config.hidden, 1)

        def forward(self, x):
            out, _ = self.lstm(x)
            return self.head(out[:, -1, :])

    return _Lstm()


def parameter_count(config: ResidualConfig) -> int:
    """Trainable parameters of the network ``config`` describes (BP 9-32-1: 353)."""
    return int(sum(p.numel() for p in _build(config).parameters()))


def _digest(state_dict) -> str:
    h = hashlib.sha256()
    for name in sorted(state_dict):
        h.update(name.encode())
        h.update(state_dict[name].detach().cpu().numpy().astype(np.float32).tobytes())
    return h.hexdigest()


def _device(config: ResidualConfig) -> str:
    """The torch device ``config`` asks for; an InputError naming ``device`` where it asks for an absent GPU."""
    torch = _torch()
    if config.device == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if config.device == "cuda" and not torch.cuda.is_available():
        raise InputError("{device} == 'cuda', but no CUDA device is available (cpu or auto train without one)",
                         fields=("device",))
    return config.device


class ResidualNetwork:
    """A trained (or loaded) residual network; ``window`` and ``predict_residual_s`` serve the chain."""

    def __init__(self, config: ResidualConfig = ResidualConfig()):
        self.config = config

    @property
    def window(self) -> int:
        return int(self.config.window)

    def fit(self, X, y_ns, X_val, y_val_ns) -> "ResidualNetwork":
        """Train on ``X`` (n, window, 9), targets ``y_ns`` (n,) in ns; early stopping on the validation
        split. Sets ``model_``, ``history_`` (per-epoch train/validation MSE, ns^2), ``train_seconds_``,
        ``device_``. Returns self."""
        torch = _torch()
        cfg = self.config
        X, X_val = self._check_inputs(X, "X"), self._check_inputs(X_val, "X_val")
        torch.manual_seed(cfg.seed)
        torch.set_num_threads(1)  # a 353-parameter network gains nothing from threads; others share the cores
        device = _device(cfg)
        model = _build(cfg).to(device)
        opt = torch.optim.Adam(model.parameters(), lr=cfg.learning_rate)
        xt = torch.as_tensor(self._shape(X), dtype=torch.float32, device=device)
        yt = torch.as_tensor(np.asarray(y_ns, dtype=np.float32)[:, None], device=device)
        xv = torch.as_tensor(self._shape(X_val), dtype=torch.float32, device=device)
        yv = torch.as_tensor(np.asarray(y_val_ns, dtype=np.float32)[:, None], device=device)
        weights = [p for n, p in model.named_parameters() if "weight" in n]
        rng = np.random.default_rng(cfg.seed)
        best, best_state, waited, history = np.inf, None, 0, []
        start = time.perf_counter()
        for _ in range(int(cfg.epochs)):
            model.train()
            order = torch.as_tensor(rng.permutation(len(xt)), device=device)
            total = 0.0
            for i in range(0, len(xt), int(cfg.batch)):
                idx = order[i:i + int(cfg.batch)]
                opt.zero_grad()
                mse = torch.mean((model(xt[idx]) - yt[idx]) ** 2)
                loss = mse + cfg.l2 * sum(torch.sum(w * w) for w in weights)  # the paper's eq. (44)
                loss.backward()
                opt.step()
                total += float(mse.detach()) * len(idx)
            model.eval()
            with torch.no_grad():
                val = float(torch.mean((model(xv) - yv) ** 2))
            history.append((total / len(xt), val))
            if val < best - 1e-6:
                best, waited = val, 0
                best_state = {k: v.detach().clone() for k, v in model.state_dict().items()}
            else:
                waited += 1
                if waited >= int(cfg.patience):
                    break
        model.load_state_dict(best_state)
        self.train_seconds_ = time.perf_counter() - start
        self.device_ = device
        self.history_ = history
        self._set_model(model.cpu())
        return self

    def _check_inputs(self, X, name):
        X = np.asarray(X, dtype=np.float64)
        want = (self.window, len(self.config.features))
        if X.ndim != 3 or X.shape[1:] != want:
            raise ValueError(f"{name} has shape {X.shape}, must be (n, {want[0]}, {want[1]})")
        return X

    def _shape(self, X):
        return X[:, 0, :] if self.config.kind == "bp" else X

    def _set_model(self, model) -> None:
        model.eval()
        self.model_ = model
        self.digest_ = _digest(model.state_dict())  # SHA-256 of the weights: names a model file's content
        self.parameter_count_ = int(sum(p.numel() for p in model.parameters()))
        if self.config.kind == "bp":
            sd = model.state_dict()
            self._w1 = sd["0.weight"].numpy().astype(np.float64)
            self._b1 = sd["0.bias"].numpy().astype(np.float64)
            self._w2 = sd["2.weight"].numpy().astype(np.float64)[0]
            self._b2 = float(sd["2.bias"].numpy()[0])

    def predict_ns(self, X) -> np.ndarray:
        """Predicted residuals (n,), ns, for inputs (n, window, 9)."""
        if not hasattr(self, "model_"):
            raise RuntimeError("this ResidualNetwork is not fitted yet: call fit() or load it")
        X = self._check_inputs(X, "X")
        if self.config.kind == "bp":
            return np.tanh(X[:, 0, :] @ self._w1.T + self._b1) @ self._w2 + self._b2  # eqs. (39)-(43)
        torch = _torch()
        with torch.no_grad():
            return self.model_(torch.as_tensor(X, dtype=torch.float32)).numpy()[:, 0].astype(np.float64)

    def predict_residual_s(self, history) -> np.ndarray:
        """The chain's call: residuals (trials,), s, from the last ``window`` exchanges' inputs."""
        return self.predict_ns(history) * 1e-9

    def save(self, path, *, training: dict | None = None) -> Path:
        """Write configuration, weights and their digest to ``path``; ``training`` (e.g. the command and seed
        that trained it) is kept with them and read back as ``training_``."""
        torch = _torch()
        sd = self.model_.state_dict()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        torch.save({"format": _FORMAT, "config": {**asdict(self.config), "features": list(self.config.features)},
                    "state_dict": sd, "digest": _digest(sd), "training": dict(training or {})}, path)
        self.training_ = dict(training or {})
        return path


def load_residual_network(path, *, chain: dict | None = None) -> ResidualNetwork:
    """Load a model file; refuse (``ChronofuseError`` naming the file) one whose weights do not match
    its configuration, whose digest differs, or (given ``chain``) that was trained behind another chain."""
    torch = _torch()
    path = Path(path)
    try:
        doc = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise
    except Exception as exc:  # torch raises several types for a file that is not a model
        raise ChronofuseError(f"{path}: not a chronofuse residual-network file ({type(exc).__name__})") from None
    if not isinstance(doc, dict) or doc.get("format") != _FORMAT or "config" not in doc or "state_dict" not in doc:
        raise ChronofuseError(f"{path}: not a chronofuse residual-network file (format {_FORMAT} expected)")
    names = {f.name for f in fields(ResidualConfig)}
    if set(doc["config"]) != names:
        raise ChronofuseError(f"{path}: its configuration has fields {sorted(doc['config'])}, expected {sorted(names)}")
    try:
        config = ResidualConfig(**doc["config"])
    except (TypeError, ValueError) as exc:
        raise ChronofuseError(f"{path}: invalid configuration ({exc})") from None
    if tuple(config.features) != FEATURES:
        raise ChronofuseError(f"{path}: trained on inputs {list(config.features)}, this version uses {list(FEATURES)}")
    model = _build(config)
    try:
        model.load_state_dict(doc["state_dict"], strict=True)
    except RuntimeError as exc:
        first = str(exc).splitlines()[0]
        raise ChronofuseError(f"{path}: the weights do not match the configuration stored with them ({first})") from None
    if _digest(model.state_dict()) != doc.get("digest"):
        raise ChronofuseError(f"{path}: the weights' digest does not match the one stored with them")
    if chain is not None and dict(config.chain) != dict(chain):
        raise ChronofuseError(f"{path}: trained behind chain {config.chain}, asked to serve {chain}")
    net = ResidualNetwork(config)
    net._set_model(model)
    net.training_ = dict(doc.get("training") or {})  # files written before it was kept: {}
    return net

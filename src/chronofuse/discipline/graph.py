"""A graph model of the receivers that outputs fusion weights (the GNSSDO paper section 4): an option.

The source paper's "graph neural network" weighs sensors by their learnt relations. Here the receivers are the
nodes of a complete graph; each second, node ``j`` carries features of what it reports and how it
agrees with the others: ``ln GDOP``, satellites / 10, the usable flag, its residual against the mean of
the other usable receivers (ns / 10) and the log of that residual's exponentially weighted mean square
(60 s memory, causal). One round of message passing (Gilmer et al., "Neural message passing for quantum
chemistry", ICML 2017)::

    h_j = MLP_1(f_j);  m_j = mean_{i != j} h_i;  logit_j = MLP_2([h_j, m_j]);  w = softmax over usable j

gives weights that sum to 1, so the fused offset ``sum_j w_j z_j`` passes the oscillator's phase
unchanged. Training is explicitly supervised with the simulated truth: it minimises the mean square of
the fused reference error ``sum_j w_j e_j`` over simulated runs (PyTorch, Adam; CPU by default, a GPU when
one is present). Whether it beats inverse-variance fusion on held-out scenarios is measured, not assumed.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from chronofuse.validation import check_array

__all__ = ["GraphFusion", "receiver_features"]

N_FEATURES = 5


def receiver_features(z, usable, gdop, n_sats, memory_s: float = 60.0) -> np.ndarray:
    """Node features (steps, receivers, 5) from offsets ``z`` and reports, all (receivers, steps); causal."""
    z = check_array(z, "z", ndim=2, allow_nan=True)
    usable = np.asarray(usable, dtype=bool) & np.isfinite(z)
    zz = np.where(usable, z, 0.0)
    n = usable.sum(axis=0, keepdims=True)
    others = np.where(n - usable > 0, (zz.sum(axis=0, keepdims=True) - zz) / np.maximum(n - usable, 1), np.nan)
    resid = np.where(usable & np.isfinite(others), zz - np.nan_to_num(others), 0.0)
    alpha = 1.0 / memory_s
    ms = lfilter([alpha], [1.0, -(1.0 - alpha)], resid**2, axis=1)
    g = np.asarray(gdop, dtype=np.float64)
    f = np.stack([np.where(np.isfinite(g), np.log(np.where(np.isfinite(g), g, 1.0)), 0.0),
                  np.asarray(n_sats, dtype=np.float64) / 10.0,
                  usable.astype(np.float64),
                  resid / 10e-9,
                  np.log(ms / 1e-18 + 1.0)], axis=-1)
    return np.transpose(f, (1, 0, 2)).astype(np.float32)


class GraphFusion:
    """Message-passing fusion weights; ``fit`` on simulated runs, ``weights``/``fuse`` on new ones.

    Parameters: ``hidden`` units, training ``epochs`` (full-batch Adam steps), ``lr``, ``seed``,
    ``device`` (None: CUDA when available, else CPU), ``max_rows`` (seconds used for training).
    Learnt: ``model_``, ``train_loss_``.
    """

    def __init__(self, hidden: int = 16, epochs: int = 200, lr: float = 1e-2, seed: int = 0, device: str | None = None,
                 max_rows: int = 8000):
        self.hidden = hidden
        self.max_rows = max_rows
        self.epochs = epochs
        self.lr = lr
        self.seed = seed
        self.device = device

    def _net(self, torch):
        h = int(self.hidden)
        nn = torch.nn

        class Net(nn.Module):
            def __init__(self):
                super().__init__()
                self.node = nn.Sequential(nn.Linear(N_FEATURES, h), nn.Tanh(), nn.Linear(h, h), nn.Tanh())
                self.out = nn.Sequential(nn.Linear(2 * h, h), nn.Tanh(), nn.Linear(h, 1))

            def forward(self, f, mask):
                hj = self.node(f)  # (B, R, h)
                count = mask.sum(dim=1, keepdim=True).clamp(min=1.0)
                total = (hj * mask[..., None]).sum(dim=1, keepdim=True)
                others = (total - hj * mask[..., None]) / (count[..., None] - mask[..., None]).clamp(min=1.0)
                logits = self.out(torch.cat([hj, others], dim=-1))[..., 0]
                logits = logits.masked_fill(mask < 0.5, -1e9)
                return torch.softmax(logits, dim=1) * (mask.sum(dim=1, keepdim=True) > 0)

        return Net()

    def fit(self, features: np.ndarray, usable: np.ndarray, errors_s: np.ndarray) -> GraphFusion:
        """Train on features (N, R, 5), usable (N, R) and the truth ``errors_s`` (N, R) (supervised).

        At most ``max_rows`` seconds (a seeded random subset) enter the full-batch training."""
        from chronofuse.extras import require

        torch = require("torch", "the graph-model fusion")

        torch.manual_seed(int(self.seed))
        device = self.device or ("cuda" if torch.cuda.is_available() else "cpu")
        keep = np.asarray(usable).any(axis=1)
        rows = np.flatnonzero(keep)
        if rows.size > self.max_rows:
            rows = np.sort(np.random.default_rng(self.seed).choice(rows, self.max_rows, replace=False))
        keep = np.zeros(keep.shape, dtype=bool)
        keep[rows] = True
        f = torch.tensor(features[keep], device=device)
        mask = torch.tensor(np.asarray(usable)[keep], dtype=torch.float32, device=device)
        e = torch.tensor(np.where(np.asarray(usable)[keep], errors_s[keep], 0.0) / 1e-9, dtype=torch.float32,
                         device=device)
        model = self._net(torch).to(device)
        opt = torch.optim.Adam(model.parameters(), lr=self.lr)
        for _ in range(int(self.epochs)):
            opt.zero_grad()
            loss = ((model(f, mask) * e).sum(dim=1) ** 2).mean()
            loss.backward()
            opt.step()
        self.model_ = model.to("cpu").eval()
        self.train_loss_ = float(loss.detach().cpu())
        return self

    def weights(self, features: np.ndarray, usable: np.ndarray) -> np.ndarray:
        """Fusion weights (N, R), summing to 1 over usable receivers (0 where none is usable)."""
        import torch

        if not hasattr(self, "model_"):
            raise RuntimeError("this GraphFusion is not fitted yet: call fit() first")
        with torch.no_grad():
            w = self.model_(torch.tensor(features), torch.tensor(np.asarray(usable), dtype=torch.float32))
        return w.numpy().astype(np.float64)

    def fuse(self, z, features: np.ndarray, usable: np.ndarray) -> np.ndarray:
        """Fused offsets (steps,) of ``z`` and ``usable`` (receivers, steps); NaN where no receiver is usable."""
        u = np.asarray(usable, dtype=bool).T
        w = self.weights(features, u)
        zz = np.where(u, np.asarray(z).T, 0.0)
        return np.where(u.any(axis=1), (w * zz).sum(axis=1), np.nan)

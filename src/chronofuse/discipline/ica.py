"""FastICA preprocessing of the multi-receiver offsets (the GNSSDO paper section 3.1, eq. (2-1)): an option.

The source paper separates the receivers' observations ``X = A S`` into independent sources by maximising the
kurtosis ``K(u) = E{u^4} / E{u^2}^2 - 3`` of ``U = W X``. Here ``X`` is the (receivers, steps) matrix of
offsets ``z_j = x - e_j``; the oscillator's phase ``x`` is common to every row, the receivers' errors
``e_j`` are not. FastICA (scikit-learn, ``fun="cube"``: the kurtosis contrast of Hyvarinen and Oja 2000)
is fitted on the first differences (stationary, where ``x``'s increments and the ``e_j``'s are mixed
instantaneously). The unmixing row whose mixing column is most nearly common to all receivers (closest
to the all-ones direction) is the common-mode extractor; normalised to sum 1 it is a set of fusion
weights ``w`` that passes ``x`` unchanged (``w . 1 = 1``) and weighs the receivers by what ICA learnt.
With ``R`` observations of ``R + 1`` sources the separation cannot be exact; whether it helps over
inverse-variance fusion is measured (``tests/discipline/test_learned_fusion.py``, docs/gnssdo), not assumed.
"""

from __future__ import annotations

import warnings

import numpy as np
from sklearn.decomposition import FastICA
from sklearn.exceptions import ConvergenceWarning

from chronofuse.validation import check_array

__all__ = ["IcaFusion"]


class IcaFusion:
    """Fusion weights from FastICA: ``fit(z)`` on training offsets (receivers, steps), ``fuse(z)`` applies them.

    Learnt: ``weights_`` (receivers,), ``unmixing_`` (receivers, receivers), ``common_index_``, ``n_iter_`` and
    ``converged_`` (whether FastICA met ``tol`` within ``max_iter``: with more sources than observations it
    may not, which a user cannot act on, so it is recorded here instead of warned about).
    """

    def __init__(self, random_state: int = 0, max_iter: int = 2000, tol: float = 1e-3):
        self.random_state = random_state
        self.max_iter = max_iter
        self.tol = tol

    def fit(self, z) -> IcaFusion:
        z = check_array(z, "z", ndim=2)
        receivers = z.shape[0]
        if receivers < 2:
            raise ValueError(f"z has {receivers} receiver(s), ICA needs at least 2")
        d = np.diff(z, axis=1).T
        ica = FastICA(n_components=receivers, fun="cube", whiten="unit-variance", random_state=self.random_state,
                      max_iter=self.max_iter, tol=self.tol)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            ica.fit(d)
        self.n_iter_ = int(ica.n_iter_)
        self.converged_ = self.n_iter_ < self.max_iter
        mixing = ica.mixing_
        align = np.abs(mixing.sum(axis=0)) / (np.sqrt(receivers) * np.linalg.norm(mixing, axis=0))
        c = int(np.argmax(align))
        w = ica.components_[c]
        self.unmixing_ = ica.components_
        self.common_index_ = c
        self.weights_ = w / w.sum()
        return self

    def fuse(self, z) -> np.ndarray:
        """``w . z`` per step: shape (steps,) for (receivers, steps)."""
        if not hasattr(self, "weights_"):
            raise RuntimeError("this IcaFusion is not fitted yet: call fit() first")
        z = check_array(z, "z", ndim=2)
        return self.weights_ @ z

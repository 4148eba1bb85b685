"""Estimation: the one layer every filter, servo, detector and sync algorithm is built on.

* :mod:`~chronofuse.estimation.interface`: the ``fit``/``reset``/``step``/``run`` contract, frozen read-only
  results, and the streaming-equals-batch checker;
* :mod:`~chronofuse.estimation.kalman`: the pure predict/update core on (N, n) states and (N, n, n) covariances;
* :mod:`~chronofuse.estimation.kalman_kernel`: its compiled twin for one state (numba), which the servos and the
  two-way link filters call in their sequential loops;
* :mod:`~chronofuse.estimation.filter`: a linear Kalman filter on the interface;
* :mod:`~chronofuse.estimation.rts`: the Rauch–Tung–Striebel smoother;
* :mod:`~chronofuse.estimation.process`: discrete process models (clock ``Phi``, ``Q``; the second difference);
* :mod:`~chronofuse.estimation.null`: the null estimator (last value held).
"""

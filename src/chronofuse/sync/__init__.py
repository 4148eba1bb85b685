"""Two-way clock synchronization over radio links (the swarm paper: Chen, Han, Yang, Xiong and Cao, J. Data
Acquisition and Processing 41(1), 2026) and the swarm's time-keeping.

* :mod:`~chronofuse.sync.base`: the one interface (the :mod:`chronofuse.estimation` contract) and the null baseline;
* :mod:`~chronofuse.sync.measurement`: the complete two-way measurement model every part below shares;
* :mod:`~chronofuse.sync.prior`, :mod:`~chronofuse.sync.calibration`: the link's stated prior, and the URT
  calibration under GNSS with its uncertainty;
* :mod:`~chronofuse.sync.pcrb`: the Bayesian bound of that prior and model;
* :mod:`~chronofuse.sync.doppler`: ``doppler-kf``, the filter on the complete model (numba loop:
  :mod:`~chronofuse.sync.doppler_kernel`), with :mod:`~chronofuse.sync.monitor` (URT changes) and
  :mod:`~chronofuse.sync.states` (the node's state);
* :mod:`~chronofuse.sync.twoway`: closed-form offsets of one exchange (the paper's eqs. 1, 9, 18; IEEE 1588);
* :mod:`~chronofuse.sync.ptp`: PTP with linuxptp's moving-median delay filter and PI servo;
* :mod:`~chronofuse.sync.regression`: linuxptp's linreg servo and a chrony-style runs-test regression;
* :mod:`~chronofuse.sync.mls`: PTP-MLS (moving least squares);
* :mod:`~chronofuse.sync.rvc`: RTT-RVC (the paper's eq. 9, and its exact-light-time form);
* :mod:`~chronofuse.sync.urt`: URT compensation, the paper's batch mode and the calibrated one;
* :mod:`~chronofuse.sync.chain`: the paper's chain ``rtt-rvc-kf`` (numba: :mod:`~chronofuse.sync.fast`);
* :mod:`~chronofuse.sync.residual`: the BP 9-32-1 residual network and the LSTM baseline (PyTorch);
* :mod:`~chronofuse.sync.metrics`: RMSE with intervals, ratios to the bound, the paper's eqs. 47-51, time error;
* :mod:`~chronofuse.sync.swarm`: neighbour graphs, leader election, the nodes' times, holdover;
* :mod:`~chronofuse.sync.registry`: the algorithms by name (:data:`~chronofuse.sync.registry.SYNC`).
"""

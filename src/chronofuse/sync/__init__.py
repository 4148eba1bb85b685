"""Two-way clock synchronization over radio links (SPEC 5, seed 001).

* :mod:`~chronofuse.sync.base`: the one interface (the :mod:`chronofuse.estimation` contract) and the null baseline;
* :mod:`~chronofuse.sync.twoway`: closed-form offsets of one exchange (seed eqs. 1, 9, 18; IEEE 1588);
* :mod:`~chronofuse.sync.ptp`: PTP with linuxptp's moving-median delay filter and PI servo;
* :mod:`~chronofuse.sync.regression`: linuxptp's linreg servo and a chrony-style runs-test regression;
* :mod:`~chronofuse.sync.mls`: PTP-MLS (moving least squares);
* :mod:`~chronofuse.sync.rvc`: RTT-RVC (seed eq. 9, and its exact-light-time form);
* :mod:`~chronofuse.sync.urt`: URT compensation, the seed's "paper" mode and the calibrated fix;
* :mod:`~chronofuse.sync.chain`: the seed's proposed chain and our Doppler-observing filters;
* :mod:`~chronofuse.sync.fast`: the seed chain's streaming step as one numba kernel (numpy twin: the chain);
* :mod:`~chronofuse.sync.network`: the BP 9-32-1 residual network and the LSTM baseline (PyTorch);
* :mod:`~chronofuse.sync.pcrb`: the posterior Cramér–Rao bound of a moving two-way link;
* :mod:`~chronofuse.sync.metrics`: RMSE, convergence epochs, robustness, overhead (seed eqs. 47-51);
* :mod:`~chronofuse.sync.registry`: algorithms by name, configured from a link model.
"""

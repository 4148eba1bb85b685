"""chronofuse: precision timing toolkit.

Truth models (oscillators, GNSS timing receivers), clock stability analysis and clock-bias integrity
monitoring. SI units inside (seconds, fractional frequency, metres, Hz); nanoseconds only at the edges.
The public surface is :mod:`chronofuse.api`.
"""

__version__ = "0.1.0"

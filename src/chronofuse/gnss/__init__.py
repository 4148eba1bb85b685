"""GNSS signal models: broadcast ephemeris, geodesy, atmosphere, observables, single-point positioning.

Below the truth models and above ``io/``: these modules take the navigation and observation records as
data (``io/rinex.py`` builds them from files) and never read files themselves.
"""

"""Figures and report folders."""

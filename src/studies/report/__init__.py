"""Figures and pages written for people: run plots and comparison reports."""

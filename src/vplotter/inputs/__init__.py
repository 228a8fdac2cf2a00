"""Inputs: readers that turn a file into records for the one shared pipeline (G-code, SVG)."""

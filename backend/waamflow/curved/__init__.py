"""Curved parts with variable-height layers (Rauch et al. 2021): fan slicing about an axis, the
bead-height model and its inverse, feasibility (CSratio) and the slicing-radius search.
"""

"""Process intelligence: coverage of sections by beads, bead models fitted from trials, parameters
filled from models, deposit compensation, interpass control and treatment paths (issue 16)."""

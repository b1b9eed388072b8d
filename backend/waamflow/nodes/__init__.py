"""Node declarations: one module per stage of the pipeline. Each is a thin adapter over a kernel.

Every module here is imported by `waamflow.engine.node.load_nodes()`.
"""

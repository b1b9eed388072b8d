"""A test node that takes its time (registered when a test imports this module; the kill -9 test
imports it into a server subprocess)."""

import time

from pydantic import Field

from waamflow.engine.node import LayerNode, NodeParams, Port, register


@register
class ToySlow(LayerNode):
    """Sleeps `seconds` per layer (checks cancel) and passes the layer on."""

    type = "toy-slow"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        seconds: float = Field(0.05, ge=0)

    def run_layer(self, ctx, params, index, items):
        t0 = time.monotonic()
        while time.monotonic() - t0 < params.seconds:
            ctx.check_cancelled()
            time.sleep(0.01)
        return {"layers": items["layers"]}

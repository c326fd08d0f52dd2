"""The contract every benchmark's ``--quick`` run keeps (no timing asserts).

A readable table first, then exactly one line of JSON, the same figures ``main`` returns;
the named figures are positive, finite floats.
"""

import json
import math


def quick_figures(module, capsys, required=()) -> dict:
    """Run ``module.main(["--quick"])``, check the contract, return the JSON figures."""
    returned = module.main(["--quick"])
    lines = capsys.readouterr().out.rstrip("\n").split("\n")
    assert sum(line.startswith("{") for line in lines) == 1
    figures = json.loads(lines[-1])
    if returned is not None:
        assert figures == json.loads(json.dumps(returned, sort_keys=True))
    for key in required:
        assert isinstance(figures[key], float), key
        assert math.isfinite(figures[key]) and figures[key] > 0, (key, figures[key])
    return figures

"""sorted_unique: the distinct values of an integer array, as np.unique gives them."""

import numpy as np
import pytest

from motes._unique import sorted_unique


@pytest.mark.parametrize("size", [0, 1, 2, 17, 5000])
def test_matches_numpy_unique(size):
    values = np.random.default_rng(size).integers(-50, 50, size)
    result = sorted_unique(values)
    np.testing.assert_array_equal(result, np.unique(values))
    assert result.dtype == values.dtype


def test_leaves_its_input_alone():
    values = np.array([3, 1, 3, 2], dtype=np.int64)
    sorted_unique(values)
    np.testing.assert_array_equal(values, [3, 1, 3, 2])

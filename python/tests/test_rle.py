import unittest

import numpy as np

from solid_data import rle


class RleTest(unittest.TestCase):
    def test_hand_computed_strings(self):
        # Worked out by hand from pycocotools' rleToString: 40 takes two characters, the
        # fourth run is stored as 2 - 40 = -38 ("jN": sign bit in the last group).
        self.assertEqual(rle.runs("0X1:jN").tolist(), [0, 40, 10, 2])
        self.assertEqual(rle.encode(np.ones((3, 4))), "0<")
        self.assertEqual(rle.encode(np.zeros((2, 2))), "4")
        # Column-major: [[0, 1], [1, 0]] is 0, 1, 1, 0.
        self.assertEqual(rle.encode(np.array([[0, 1], [1, 0]])), "121")
        np.testing.assert_array_equal(rle.decode("121", 2, 2), [[0, 1], [1, 0]])

    def test_round_trip_random_masks(self):
        rng = np.random.default_rng(1)
        for trial in range(200):
            h, w = (int(v) for v in rng.integers(1, 60, 2))
            if trial % 2:
                mask = (rng.random((h, w)) < rng.random()).astype(np.uint8)
            else:  # long runs, so that values take several characters and deltas go negative
                mask = np.zeros((h, w), np.uint8)
                mask[rng.integers(0, h):, rng.integers(0, w):] = 1
            counts = rle.encode(mask)
            np.testing.assert_array_equal(rle.decode(counts, h, w), mask)
            self.assertEqual(rle.area(counts), int(mask.sum()))

    def test_bbox(self):
        mask = np.zeros((5, 7), np.uint8)
        mask[1:3, 2:6] = 1
        self.assertEqual(rle.bbox(mask), (2, 1, 4, 2))
        self.assertEqual(rle.bbox(np.zeros((3, 3))), (0, 0, 0, 0))

    def test_rejects_malformed(self):
        with self.assertRaises(ValueError):
            rle.decode("4", 2, 3)  # covers 4 pixels of 6
        with self.assertRaises(ValueError):
            rle.runs("X")  # continuation flag on the last character
        with self.assertRaises(ValueError):
            rle.runs("1~")


if __name__ == "__main__":
    unittest.main()

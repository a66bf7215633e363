import unittest

try:
    from torch.distributed.elastic.multiprocessing import Std

    from solid_data.launch import parse_std
except ImportError as error:
    raise unittest.SkipTest(f"PyTorch is not importable: {error}")


class ParseStdTest(unittest.TestCase):
    def test_torchruns_defaults_and_maps_parse_by_value(self):
        self.assertIs(parse_std("0"), Std.NONE)
        self.assertIs(parse_std("3"), Std.ALL)
        self.assertEqual(parse_std("0:3,1:0"), {0: Std.ALL, 1: Std.NONE})
        with self.assertRaises(ValueError):
            parse_std("all")


if __name__ == "__main__":
    unittest.main()

"""Reading solid datasets from Python: sqlite3, NumPy and Pillow; `solid_data.torch` adds PyTorch."""

from .dataset import Dataset, Image, Instance, QueryView, decode_image

__all__ = ["Dataset", "Image", "Instance", "QueryView", "decode_image"]

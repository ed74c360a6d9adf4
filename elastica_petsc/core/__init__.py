"""core"""
# registers the kernel of cables through guides, offsets and weight with
# Discretisation.from_arm (docs/model.md §11)
from . import guided  # noqa: F401

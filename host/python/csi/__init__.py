"""csi: compressive signal integration from Python.

Importing the package needs only numpy; the parts that call the C library load it when first
used, and the renderer bridges import their renderer only when they run.
"""

__version__ = "0.1.0"

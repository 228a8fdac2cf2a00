"""vplotter: drive a hanging wall plotter (V-plotter) from a Raspberry Pi."""

__version__ = "0.1.0"

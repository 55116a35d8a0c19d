"""dresslog: simulate robot-assisted dressing, record trials to MCAP, infer applied forces."""

__version__ = "0.1.0"

__all__ = ["__version__"]

"""Converters: external robot logs (ROS 1/2 bags, MCAP, force/torque CSV) into dresslog trials."""

from dresslog.convert.convert import ConversionReport, ConversionWarning, convert, load

__all__ = ["ConversionReport", "ConversionWarning", "convert", "load"]

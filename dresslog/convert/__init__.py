"""Converters: external robot logs (ROS 1/2 bags, MCAP, force/torque CSV) into dresslog trials."""

from dresslog.convert.convert import ConversionReport, ConversionWarning, convert, load
from dresslog.convert.options import ConvertOptions
from dresslog.convert.signal import OptionError, SignalOptions

__all__ = [
    "ConversionReport",
    "ConversionWarning",
    "ConvertOptions",
    "OptionError",
    "SignalOptions",
    "convert",
    "load",
]

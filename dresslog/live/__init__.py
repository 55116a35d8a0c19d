"""`dresslog live`: the force map from a robot's ROS 2 stream, estimated as it arrives.

`LiveSession` (no ROS) resamples, places and estimates; `ros` wraps it in an rclpy node;
`run_live` is the command as a library call.
"""

from dresslog.live.options import LiveOptions
from dresslog.live.run import LiveReport, run_live
from dresslog.live.session import LiveSession, LiveWarning

__all__ = ["LiveOptions", "LiveReport", "LiveSession", "LiveWarning", "run_live"]

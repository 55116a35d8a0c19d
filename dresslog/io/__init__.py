"""The trial file: MCAP (profile ros2, CDR) read and written with typed ROS 2 messages.

`writer.TrialWriter` and `reader.TrialReader` (context managers) are the only ways in and
out; `cdr` is the numpy codec compiled from `schemas/` (`msgdefs`), `well_known` names
the topics and types, `files` writes atomically, `summary` describes a trial for `info`.
"""

"""Recording the robot's run to MCAP, serving it live to Foxglove, and playing it back (issue 18).

`Recorder` takes the daemon's messages without blocking (a bounded queue and a writer thread),
converts them to Foxglove's well-known schemas and writes rotating MCAP files and/or a live
Foxglove WebSocket server. `replay` reads a recording back and plays it as a robot on zenoh.
"""

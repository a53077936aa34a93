"""Running a certified law on vehicles: the runtime law, the MAVLink link, the monitor, the loop, logs and replay."""

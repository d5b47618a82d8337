"""What this computer offers, in one place: the operating system (`host`: shared memory, process watches,
file locks), serial ports (`ports`, `servo_port`), per-device files (`calibration_files`), the keys of
multi-machine stations (`keys`) and two network namespaces joined as two machines for tests (`netns`).

A floor just above `rio.errors`: it knows nothing of nodes, plugins or stations, so every other part of
RIO may use it (docs/architecture.md).
"""

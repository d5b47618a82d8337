"""What this computer offers, in one place: the operating system (`host`: shared memory, process watches,
file locks), serial ports (`ports`, `servo_port`), per-device files (`calibration_files`), the keys of
multi-machine stations (`keys`), two network namespaces joined as two machines for tests (`netns`), the
one check that a name read from a shared file stays inside its directory (`confine`), and the share of
numbered resources (loopback addresses, DDS domains) a parallel test worker draws from (`parallel`).

A floor just above `rio.errors`: it knows nothing of nodes, plugins or stations, so every other part of
RIO may use it (docs/architecture.md).
"""

"""The node runtime: the bottom floor every other part of RIO stands on.

A node (`node`) declares its samples and requests, whose fixed binary layout (`layout`) gives the ring
buffers and request queues (`buffers`, checked slots: `slot_check`, recycled copies: `recycle`) and the
wire format (`wire`). `runner` runs a node's loops; `manager` serves nodes in processes or threads and makes
their clients (`client`); `transport` is the interface every middleware implements; `ring_ref` names a ring
so another local consumer reads it in place; `peer` hands a node a reference from which it connects its own
client of another node; `sweep` removes what killed runs left behind; `top` reads the
running stations of this machine. Nothing here imports a middleware backend, a plugin, a station or a
workflow (docs/architecture.md); the public names are re-exported by `rio` itself (`from rio import serve`).
"""

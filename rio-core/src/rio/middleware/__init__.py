"""Middlewares: how a node's state, requests and API calls travel between server and client."""

from rio.runtime.transport import ClientTransport, Middleware, MiddlewareConfig, NodeLayouts, ServerTransport

__all__ = ["Middleware", "MiddlewareConfig", "ServerTransport", "ClientTransport", "NodeLayouts"]

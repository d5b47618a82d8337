"""Middlewares: how a node's state, requests and API calls travel between server and client."""

from .base import ClientTransport, Middleware, MiddlewareConfig, NodeLayouts, ServerTransport

__all__ = ["Middleware", "MiddlewareConfig", "ServerTransport", "ClientTransport", "NodeLayouts"]

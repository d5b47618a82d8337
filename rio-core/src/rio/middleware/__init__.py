"""Middlewares: how a node's state, requests and API calls travel between server and client."""

from .base import ClientTransport, Middleware, MiddlewareOptions, NodeLayouts, ServerTransport

__all__ = ["Middleware", "MiddlewareOptions", "ServerTransport", "ClientTransport", "NodeLayouts"]

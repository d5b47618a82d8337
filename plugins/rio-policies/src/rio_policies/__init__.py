"""rio-policies: policy adapters for RIO (`rio deploy STATION --policy NAME,...`).

Each adapter is a `rio.policy.Policy` (load / prepare / infer) hosted by a `rio.policy.PolicyNode`
subclass; `rio_policies.plugin` registers them by name. Vendor libraries are imported only in
`load()`, so listing plugins never needs them.
"""

"""HTTP layer: dependencies, routers, one module of routes per resource."""

"""Services: what the routes and the CLI call; they own validation and transactions."""

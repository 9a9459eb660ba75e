"""rigidlab app: viser server and scenes that adapt core results (no physics here)."""

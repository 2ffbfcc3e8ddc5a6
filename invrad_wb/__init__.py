"""invrad."""

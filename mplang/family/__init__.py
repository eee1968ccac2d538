"""What every controller family shares: the face the CLI reaches each family through, the
registry of families, and what their virtual controllers share (traces, pty links)."""

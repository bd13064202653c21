"""Table renderers: one module per paper, one small function per table."""

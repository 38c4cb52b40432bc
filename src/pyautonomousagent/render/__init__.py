"""Phase 7: drawing recorded runs (the paper's Fig. 5 layout) and writing animated GIFs."""

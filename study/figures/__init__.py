"""Figure scripts: they draw computed results and compute nothing of their own."""

"""The analyses stage: frontiers, threshold minima, coupling effects, fits, designs,
measurements, selection and export."""

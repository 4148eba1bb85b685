"""Physical truth models: oscillators and their noise."""

"""What a match is asked to do: the option table and its presets (params), tau (tau),
the paper's settings (paper)."""

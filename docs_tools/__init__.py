"""Tools that build parts of docs/ from the code (outside the layers of ARCHITECTURE.md: nothing imports them)."""

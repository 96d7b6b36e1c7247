"""Pure numerical core: arrays in, arrays or result objects out. No files, no printing."""

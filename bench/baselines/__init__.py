"""Methods from the literature the thesis argues against, implemented as well as we would a feature."""

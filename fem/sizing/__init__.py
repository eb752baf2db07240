"""Model no more than a scene needs: ``fem.size_model`` and its stages, curves and report."""

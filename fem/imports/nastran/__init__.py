"""Nastran bulk-data decks solved by our own models: the cards, coordinate systems, elements,
constraints and the deck model (``fem.from_nastran``)."""

"""Models and modes from other tools' files: ANSYS, Nastran (decks, OP2, punch), Universal
Files, the preprint's R1, and the checks every imported model passes."""

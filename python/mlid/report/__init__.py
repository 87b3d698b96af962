"""What is shown of a fit: plots, the HTML page of a deck, comparison with
the textbook software's reference fits, and validation on held-out
manoeuvres (here because Validation.plot draws through plots.py)."""

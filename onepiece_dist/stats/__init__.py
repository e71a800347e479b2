"""Statistics on plain arrays (pure numpy): intervals over objects, average precision, a label's ceiling, and
which candidates to label next."""

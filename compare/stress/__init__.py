"""`rtval stress`: where each method breaks, before it misleads anyone."""

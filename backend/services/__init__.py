"""What the API computes from stored jobs: results and comparisons, weights, studies and their plots."""

"""Evaluation against ground truth: metrics, baselines, dense scores."""

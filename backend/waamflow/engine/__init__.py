"""The dataflow engine: node declarations, recipes, validation, signature cache, execution."""

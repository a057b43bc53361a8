"""The Sidewalk modules: vocabulary, runtime, and one sub-package per module."""

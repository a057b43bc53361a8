"""The EDDIE variant: point-to-point links, controller-held position, annotated maps."""

"""Signal generators: CSM scintillation (and, later, dynamics, correlators, jamming)."""

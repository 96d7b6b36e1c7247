"""trms-ident: DREM parameter identification for the Twin Rotor MIMO System."""
__version__ = "0.1.0"

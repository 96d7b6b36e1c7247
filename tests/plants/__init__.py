"""Test plants written independently of sim/ and trms_ident/: published TRMS models, ported from their equations."""

"""Offline tools: ``cyborgd analyze`` on saved images, and the paper's reproduction."""

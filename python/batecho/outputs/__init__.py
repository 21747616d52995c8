"""What results are written as: NPZ files with the settings that reproduce them
(:mod:`~batecho.outputs.npz`), and figures of echoes, scenes, trees and forests (matplotlib,
loaded on first use)."""

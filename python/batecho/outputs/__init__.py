"""What results are written as: figures of echoes, scenes, trees and forests (matplotlib,
loaded on first use)."""

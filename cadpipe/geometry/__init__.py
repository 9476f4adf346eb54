"""The geometry chain: path -> frames and rings -> pipe -> splice -> mesh.

Plain values and functions over arrays; nothing here reads or writes files.
"""

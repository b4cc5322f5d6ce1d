"""The built-in environment adapters: highway, frozenlake, cliffwalking."""

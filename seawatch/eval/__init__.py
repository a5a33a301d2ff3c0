"""seawatch.eval"""

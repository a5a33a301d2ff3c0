"""seawatch.train"""

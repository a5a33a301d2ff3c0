"""seawatch.detect"""
